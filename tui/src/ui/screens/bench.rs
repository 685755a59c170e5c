//! The Bench screen: each device with its state (axes: position, homed, moving, soft limits,
//! faults; F/T: force, rate, lost samples; camera: fps, drops), the chosen axis and jog step,
//! the force over the last seconds, the newest frame and what the bench said.

use crate::ui::app::App;
use crate::ui::binding::{self, char, code, Binding, HelpRow, Scope};
use crate::ui::picture::Picture;
use crate::ui::screen::{Screen, ScreenDef};
use crate::ui::stage_operator::UiStageOperator;
use crate::ui::state::{BenchView, Tab, JOG_STEPS_MM};
use crate::ui::widgets::time_chart::{self, Series};
use crate::ui::widgets::{panel, ACCENT, BAD, GOOD, MEASURED, WARN};
use fringe_app::session::{AxisId, AxisState, BenchCommand, BenchPhase, BenchSession, BenchState};
use fringe_rig::Millimetres;
use ratatui::crossterm::event::{KeyCode, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, Wrap};
use ratatui::Frame;

/// Side of the Bench screen's frame picture, px.
const PICTURE_PX: u32 = 96;

/// This screen, by name: `UiState::tab` when it is shown; the command line and other code
/// choose it by this.
pub const TAB: Tab = Tab::named("bench");

pub const SCREEN: ScreenDef = ScreenDef {
    tab: TAB,
    title: "Bench",
    help,
    draw: |f, area, s| draw(f, area, &s.bench),
    hint: |_| KEY_HINT,
    open: |_| Box::new(Bench),
};

/// The keys that act on the bench.
const KEY_HINT: &str = "x y z axis · ←/→ jog · s step · h home · Space stop · t tare";

#[derive(Debug, Clone, Copy)]
enum Action {
    Axis(AxisId),
    NextStep,
    Jog(f64),
    Home,
    Stop,
    Tare,
}

const KEYS: &[Binding<Action>] = &[
    Binding {
        keys: &[char('x')],
        scope: Scope::Shown,
        action: Action::Axis(AxisId::X),
        label: "x y z",
        help: "choose the axis to jog",
    },
    Binding {
        keys: &[char('y')],
        scope: Scope::Shown,
        action: Action::Axis(AxisId::Y),
        label: "",
        help: "",
    },
    Binding {
        keys: &[char('z')],
        scope: Scope::Shown,
        action: Action::Axis(AxisId::Z),
        label: "",
        help: "",
    },
    Binding {
        keys: &[code(KeyCode::Left), char('-')],
        scope: Scope::Shown,
        action: Action::Jog(-1.0),
        label: "← →",
        help: "jog the axis by the step (within its soft limits)",
    },
    Binding {
        keys: &[code(KeyCode::Right), char('+'), char('=')],
        scope: Scope::Shown,
        action: Action::Jog(1.0),
        label: "",
        help: "",
    },
    Binding {
        keys: &[char('s')],
        scope: Scope::Shown,
        action: Action::NextStep,
        label: "s",
        help: "next jog step: 0.01, 0.1, 1, 5 mm",
    },
    Binding {
        keys: &[char('h')],
        scope: Scope::Shown,
        action: Action::Home,
        label: "h",
        help: "home the chosen axis",
    },
    Binding {
        keys: &[char(' ')],
        scope: Scope::Shown,
        action: Action::Stop,
        label: "Space",
        help: "stop every axis at once",
    },
    Binding {
        keys: &[char('t')],
        scope: Scope::Shown,
        action: Action::Tare,
        label: "t",
        help: "tare the F/T (z homed first; refused in contact)",
    },
];

fn help() -> Vec<HelpRow> {
    binding::help_rows(KEYS, Some(SCREEN.title))
}

/// Opens the bench (the [`App`] holds it) while the screen is shown and no scan holds the
/// devices; closes it when another screen is (so a scan can open them).
struct Bench;

impl Screen for Bench {
    fn key(&mut self, app: &mut App, code: KeyCode, mods: KeyModifiers, shown: bool) -> bool {
        let Some(action) = binding::find(KEYS, code, mods, shown) else {
            return false;
        };
        let view = &mut app.state.bench;
        match action {
            Action::Axis(axis) => view.axis = axis,
            Action::NextStep => view.step = (view.step + 1) % JOG_STEPS_MM.len(),
            Action::Jog(sign) => {
                let by = Millimetres(sign * view.step_mm());
                let axis = view.axis;
                app.bench_command(BenchCommand::Jog { axis, by });
            }
            Action::Home => {
                let axis = view.axis;
                app.bench_command(BenchCommand::Home(axis))
            }
            Action::Stop => app.bench_command(BenchCommand::Stop),
            Action::Tare => app.bench_command(BenchCommand::Tare),
        }
        true
    }

    fn tick(&mut self, app: &mut App, shown: bool) -> bool {
        if shown && app.scan_active() {
            app.close_bench();
            app.state.bench.held = Some(
                "a scan holds the devices: its state is on the Scan screen; the bench opens \
                 here when it ends"
                    .into(),
            );
            return false;
        }
        if app.stream.is_some() {
            app.close_bench();
            app.state.bench.held = Some(
                "the stream holds the camera: stop it on the Stream screen (s) to use the bench"
                    .into(),
            );
            return false;
        }
        app.state.bench.held = None;
        if shown && app.bench.is_none() {
            app.state.bench.bench = Default::default();
            match BenchSession::open(
                app.opts.config.clone(),
                PICTURE_PX,
                Box::new(UiStageOperator),
            ) {
                Ok(b) => app.bench = Some(b),
                Err(e) => app.state.error = Some(format!("cannot start the bench thread: {e}")),
            }
        } else if !shown {
            app.close_bench();
        }
        match &app.bench {
            Some(b) => {
                app.state.bench.bench = b.state();
                true
            }
            None => false,
        }
    }
}

fn draw(f: &mut Frame, area: Rect, v: &BenchView) {
    let [left, right] =
        Layout::horizontal([Constraint::Percentage(60), Constraint::Percentage(40)]).areas(area);
    let [devices_area, chart_area] =
        Layout::vertical([Constraint::Length(10), Constraint::Min(0)]).areas(left);
    let [picture_area, log_area] =
        Layout::vertical([Constraint::Percentage(55), Constraint::Percentage(45)]).areas(right);
    draw_devices(f, devices_area, v);
    let fz: Vec<(f64, f64)> = v.bench.chart.iter().map(|p| (p.t_s, p.fz_n)).collect();
    let ft: Vec<(f64, f64)> = v.bench.chart.iter().map(|p| (p.t_s, p.f_n)).collect();
    time_chart::draw(
        f,
        chart_area,
        "force, N",
        &[
            Series {
                name: "Fz",
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
    let block = panel("camera");
    let inner = block.inner(picture_area);
    f.render_widget(block, picture_area);
    match &v.bench.picture {
        Some(p) => f.render_widget(Picture(p), inner),
        None => f.render_widget(Paragraph::new("no frame yet"), inner),
    }
    // Newest first, wrapped: a stop or a refusal is read whole.
    let lines: Vec<Line> = v
        .bench
        .messages
        .iter()
        .rev()
        .take(log_area.height.saturating_sub(2) as usize)
        .map(|m| {
            let bad = m.contains("over the ceiling")
                || m.contains("outside the soft limits")
                || m.contains("axis ")
                || m.contains(" is refused")
                || m.contains("reads a load");
            let style = if bad {
                Style::new().fg(BAD)
            } else {
                Style::new()
            };
            Line::styled(m.clone(), style)
        })
        .collect();
    f.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(panel("messages (newest first)")),
        log_area,
    );
}

/// The devices panel: the phase and jog step, the axes, the F/T sensor and the camera.
fn draw_devices(f: &mut Frame, area: Rect, v: &BenchView) {
    let (phase, colour) = phase_text(v);
    let block = panel("bench");
    let inner = block.inner(area);
    f.render_widget(block, area);
    let [status_area, table_area, lines_area] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(4),
        Constraint::Min(0),
    ])
    .areas(inner);
    f.render_widget(
        Paragraph::new(Line::from(vec![
            Span::styled(phase, Style::new().fg(colour)),
            Span::raw(format!("   jog step {} mm", v.step_mm())),
        ])),
        status_area,
    );
    f.render_widget(axis_table(v), table_area);
    f.render_widget(Paragraph::new(stream_lines(&v.bench)), lines_area);
}

/// What the bench is doing (or why it is held), and its colour.
fn phase_text(v: &BenchView) -> (String, Color) {
    match (&v.held, &v.bench.phase) {
        (Some(why), _) => (why.clone(), WARN),
        (None, BenchPhase::Opening) => ("opening the devices...".to_string(), ACCENT),
        (None, BenchPhase::Ready) => ("ready".to_string(), GOOD),
        (None, BenchPhase::Failed(e)) => (format!("failed: {e}"), BAD),
        (None, BenchPhase::Closed) => ("closed".to_string(), ACCENT),
    }
}

/// The axes, one row each, the chosen one marked and bold.
fn axis_table(v: &BenchView) -> Table<'static> {
    let rows: Vec<Row> = AxisId::ALL
        .iter()
        .zip(&v.bench.axes)
        .map(|(id, a)| {
            let chosen = *id == v.axis;
            let row = axis_row(*id, a, chosen);
            if chosen {
                row.style(Style::new().add_modifier(Modifier::BOLD))
            } else {
                row
            }
        })
        .collect();
    Table::new(
        rows,
        [
            Constraint::Length(4),
            Constraint::Length(13),
            Constraint::Length(10),
            Constraint::Length(7),
            Constraint::Length(18),
            Constraint::Min(0),
        ],
    )
    .header(
        Row::new(["axis", "position", "", "", "soft limits, mm", ""])
            .style(Style::new().add_modifier(Modifier::DIM)),
    )
}

/// One axis: position, homed, moving, soft limits and faults.
fn axis_row(id: AxisId, a: &AxisState, chosen: bool) -> Row<'static> {
    let position = a
        .position_mm
        .map_or("-".to_string(), |p| format!("{p:>9.4} mm"));
    let state = if a.manual {
        Span::raw("by hand")
    } else if a.moving {
        Span::styled("moving", Style::new().fg(WARN))
    } else {
        Span::raw("idle")
    };
    let homed = if a.homed || a.manual {
        Span::styled("homed", Style::new().fg(GOOD))
    } else {
        Span::styled("not homed", Style::new().fg(WARN))
    };
    let faults = if a.faults.is_empty() {
        Span::raw("")
    } else {
        Span::styled(a.faults.join(", "), Style::new().fg(BAD))
    };
    Row::new(vec![
        Cell::from(format!("{} {}", if chosen { "▶" } else { " " }, id.name())),
        Cell::from(position),
        Cell::from(homed),
        Cell::from(state),
        Cell::from(format!("{:.3} .. {:.3}", a.limits_mm.0, a.limits_mm.1)),
        Cell::from(faults),
    ])
}

/// The F/T sensor's force, ceiling, rate, losses and peak, and the camera's rate and drops.
fn stream_lines(b: &BenchState) -> Vec<Line<'static>> {
    let over = b.force.max_n > 0.0 && b.force.f_n > b.force.max_n;
    let lost = if b.force.lost > 0 {
        Span::styled(format!("{} lost", b.force.lost), Style::new().fg(WARN))
    } else {
        Span::raw("0 lost")
    };
    let dropped = if b.camera.dropped > 0 {
        Span::styled(
            format!("{} dropped", b.camera.dropped),
            Style::new().fg(WARN),
        )
    } else {
        Span::raw("0 dropped")
    };
    vec![
        Line::from(vec![
            Span::raw("F/T  "),
            Span::styled(
                format!("Fz {:>7.3} N  |F| {:>7.3} N", b.force.fz_n, b.force.f_n),
                Style::new().fg(if over { BAD } else { MEASURED }),
            ),
            Span::raw(format!(
                "  ceiling {:.1} N  {:>6.0} Hz  ",
                b.force.max_n, b.force.rate_hz
            )),
            lost,
        ]),
        Line::from(vec![
            Span::raw("     "),
            Span::styled(
                format!("peak |F| {:>7.3} N since opened or tared", b.force.peak_n),
                Style::new().fg(if b.force.max_n > 0.0 && b.force.peak_n > b.force.max_n {
                    WARN
                } else {
                    MEASURED
                }),
            ),
        ]),
        Line::from(vec![
            Span::raw(format!(
                "cam  {:>5.1} fps  frame {}  ",
                b.camera.fps, b.camera.frame_id
            )),
            dropped,
        ]),
    ]
}
