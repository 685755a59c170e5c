//! The Bench screen: each device with its state (axes: position, homed, moving, soft limits,
//! faults; F/T: force, rate, lost samples; camera: fps, drops), the chosen axis and jog step,
//! the force over the last seconds, the newest frame and what the bench said.

use super::time_chart::{self, Series};
use super::{panel, ACCENT, BAD, GOOD, MEASURED, WARN};
use crate::ui::picture::Picture;
use crate::ui::state::BenchView;
use fringe_app::bench_session::{AxisId, BenchPhase};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, Paragraph, Row, Table, Wrap};
use ratatui::Frame;

/// The keys that act on the bench.
pub(crate) const KEY_HINT: &str = "x y z axis · ←/→ jog · s step · h home · Space stop · t tare";

pub(crate) fn draw(f: &mut Frame, area: Rect, v: &BenchView) {
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
                || m.contains("axis ");
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

fn draw_devices(f: &mut Frame, area: Rect, v: &BenchView) {
    let b = &v.bench;
    let (phase, colour) = match (&v.held, &b.phase) {
        (Some(why), _) => (why.clone(), WARN),
        (None, BenchPhase::Opening) => ("opening the devices...".to_string(), ACCENT),
        (None, BenchPhase::Ready) => ("ready".to_string(), GOOD),
        (None, BenchPhase::Failed(e)) => (format!("failed: {e}"), BAD),
        (None, BenchPhase::Closed) => ("closed".to_string(), ACCENT),
    };
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
    let rows: Vec<Row> = AxisId::ALL
        .iter()
        .zip(&b.axes)
        .map(|(id, a)| {
            let chosen = *id == v.axis;
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
            let row = Row::new(vec![
                Cell::from(format!("{} {}", if chosen { "▶" } else { " " }, id.name())),
                Cell::from(position),
                Cell::from(homed),
                Cell::from(state),
                Cell::from(format!("{:.3} .. {:.3}", a.limits_mm.0, a.limits_mm.1)),
                Cell::from(faults),
            ]);
            if chosen {
                row.style(Style::new().add_modifier(Modifier::BOLD))
            } else {
                row
            }
        })
        .collect();
    let table = Table::new(
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
    );
    f.render_widget(table, table_area);
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
    let lines = vec![
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
    ];
    f.render_widget(Paragraph::new(lines), lines_area);
}
